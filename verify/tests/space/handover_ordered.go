// D1 holds a spot, leaves it and says so; only then does D2 fly into it.
package HandoverOrdered

var (
	D1 Quadcopter
	D2 Quadcopter
)

func PAR_Mission() {
	SEQ_First()
	SEQ_Second()
}

func SEQ_First() {
	D1.Arm()
	D1.Takeoff(5)
	D1.FlyByX(10)
	D1.Hover(2)
	D1.FlyByY(-10)
	Signal("left")
	D1.FlyByX(-10)
	D1.Land()
}

func SEQ_Second() {
	D2.Arm()
	D2.Takeoff(5)
	Await("left")
	D2.FlyTo(10, -3, 5)
	D2.Land()
}
