// A block call and a block argument that name no function.
package UnknownFunction

var Drone1 Quadcopter

func INIT() {
	SEQ_Fyl()
	RepeatFor(2, SEQ_Fli)
}

func SEQ_Fly() {
	Drone1.FlyByX(1)
}
