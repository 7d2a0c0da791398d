// Three lanes of a survey: each round moves D1 four metres east, three
// rounds in all.
package Lawnmower

var D1 Quadcopter

func SEQ_Mission() {
	D1.Arm()
	D1.Takeoff(5)
	RepeatFor(3, SEQ_Lanes)
	D1.ReturnHome()
	D1.Land()
}

func SEQ_Lanes() {
	D1.FlyByX(10)
	D1.FlyByY(2)
	D1.FlyByX(-10)
	D1.FlyByY(2)
}
